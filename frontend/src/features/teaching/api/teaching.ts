import { apiGet, apiPost } from '@/lib/api-client';

export async function setTeaching(enabled: boolean): Promise<boolean> {
  const reply = await apiPost<{ enabled: boolean }>('/api/agent/teaching', { enabled });
  return reply.enabled;
}

export async function getTeaching(): Promise<boolean> {
  return (await apiGet<{ enabled: boolean }>('/api/agent/teaching')).enabled;
}
