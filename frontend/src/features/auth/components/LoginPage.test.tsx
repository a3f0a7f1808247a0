import { render, screen, waitFor } from '@testing-library/react';
import userEvent from '@testing-library/user-event';
import { afterEach, describe, expect, it, vi } from 'vitest';
import { checkSession } from '../api/auth';
import { LoginPage } from './LoginPage';

afterEach(() => vi.unstubAllGlobals());

describe('login', () => {
  it.each([
    [401, 'signed-out'],
    [404, 'open'],
    [200, 'signed-in'],
  ])('with a login, /api/auth/me answering %i means %s', async (status, session) => {
    const config = new Response(JSON.stringify({ auth: true }), { status: 200 });
    vi.stubGlobal('fetch', vi.fn(async (url: string) => (url === '/api/ui/config' ? config : new Response('{}', { status }))));
    expect(await checkSession()).toBe(session);
  });

  it('a brain without a login is open and is never asked /api/auth/me', async () => {
    const fetchMock = vi.fn(async () => new Response(JSON.stringify({ auth: false }), { status: 200 }));
    vi.stubGlobal('fetch', fetchMock);
    expect(await checkSession()).toBe('open');
    expect(fetchMock).toHaveBeenCalledTimes(1);
  });

  it('a 401 on the config means signed out', async () => {
    vi.stubGlobal('fetch', vi.fn(async () => new Response('{}', { status: 401 })));
    expect(await checkSession()).toBe('signed-out');
  });

  it('posts the credentials and reports a refusal inline', async () => {
    const fetchMock = vi.fn(async () => new Response(JSON.stringify({ detail: 'wrong password' }), { status: 401 }));
    vi.stubGlobal('fetch', fetchMock);
    const signedIn = vi.fn();
    render(<LoginPage onSignedIn={signedIn} />);
    await userEvent.type(screen.getByLabelText('Password'), 'nope');
    await userEvent.click(screen.getByRole('button', { name: 'Sign in' }));
    await waitFor(() => expect(screen.getByRole('alert')).toHaveTextContent('wrong password'));
    expect(signedIn).not.toHaveBeenCalled();
    expect(fetchMock).toHaveBeenCalledWith('/api/auth/login', expect.objectContaining({ method: 'POST', body: JSON.stringify({ username: 'admin', password: 'nope' }) }));
  });
});
